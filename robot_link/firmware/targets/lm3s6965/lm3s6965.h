/* The few TI Stellaris LM3S6965 registers this board support uses, by
 * address (datasheet DS-LM3S6965), plus the Cortex-M3 core registers. No
 * vendor SDK: every register the code touches is named here. */
#ifndef ODOLINK_LM3S6965_H_
#define ODOLINK_LM3S6965_H_

#include <stdint.h>

#define LM3S_REG(addr) (*(volatile uint32_t*)(uintptr_t)(addr))

/* ---- Memory map ---- */
#define LM3S_FLASH_SIZE (256u * 1024u)
#define LM3S_FLASH_PAGE_SIZE 1024u
#define LM3S_SRAM_SIZE (64u * 1024u)

/* ---- System control ---- */
#define SYSCTL_RIS LM3S_REG(0x400FE050u)
#define SYSCTL_RIS_PLLLRIS (1u << 6)
#define SYSCTL_RCC LM3S_REG(0x400FE060u)
#define SYSCTL_RCC_MOSCDIS (1u << 0)
#define SYSCTL_RCC_OSCSRC_MASK (3u << 4)
#define SYSCTL_RCC_XTAL_MASK (0xFu << 6)
#define SYSCTL_RCC_XTAL_8MHZ (0xEu << 6)
#define SYSCTL_RCC_BYPASS (1u << 11)
#define SYSCTL_RCC_PWRDN (1u << 13)
#define SYSCTL_RCC_USESYSDIV (1u << 22)
#define SYSCTL_RCC_SYSDIV_MASK (0xFu << 23)
#define SYSCTL_RCC_SYSDIV(n) ((uint32_t)(n) << 23) /* PLL 200 MHz / (n + 1) */
#define SYSCTL_USECRL LM3S_REG(0x400FE140u)
#define SYSCTL_RCGC1 LM3S_REG(0x400FE104u)
#define SYSCTL_RCGC1_UART0 (1u << 0)
#define SYSCTL_RCGC2 LM3S_REG(0x400FE108u)
#define SYSCTL_RCGC2_GPIOA (1u << 0)

/* ---- GPIO port A (UART0 RX = PA0, TX = PA1) ---- */
#define GPIOA_AFSEL LM3S_REG(0x40004420u)
#define GPIOA_DEN LM3S_REG(0x4000451Cu)

/* ---- UART0: an ARM PL011 ---- */
#define UART0_BASE 0x4000C000u
#define UART0_DR LM3S_REG(UART0_BASE + 0x000u)
#define UART0_FR LM3S_REG(UART0_BASE + 0x018u)
#define UART_FR_RXFE (1u << 4)
#define UART_FR_TXFF (1u << 5)
#define UART0_IBRD LM3S_REG(UART0_BASE + 0x024u)
#define UART0_FBRD LM3S_REG(UART0_BASE + 0x028u)
#define UART0_LCRH LM3S_REG(UART0_BASE + 0x02Cu)
#define UART_LCRH_FEN (1u << 4)
#define UART_LCRH_WLEN_8 (3u << 5)
#define UART0_CTL LM3S_REG(UART0_BASE + 0x030u)
#define UART_CTL_UARTEN (1u << 0)
#define UART_CTL_TXE (1u << 8)
#define UART_CTL_RXE (1u << 9)
#define UART0_IFLS LM3S_REG(UART0_BASE + 0x034u)
#define UART0_IM LM3S_REG(UART0_BASE + 0x038u)
#define UART0_MIS LM3S_REG(UART0_BASE + 0x040u)
#define UART0_ICR LM3S_REG(UART0_BASE + 0x044u)
#define UART_INT_RX (1u << 4)
#define UART_INT_RT (1u << 6)
#define UART_INT_OE (1u << 10)
#define UART0_IRQ 5u

/* ---- Flash memory controller (used only by flash_hw_fmc.c) ---- */
#define FLASH_FMA LM3S_REG(0x400FD000u)
#define FLASH_FMD LM3S_REG(0x400FD004u)
#define FLASH_FMC LM3S_REG(0x400FD008u)
#define FLASH_FMC_WRKEY 0xA4420000u
#define FLASH_FMC_WRITE (1u << 0)
#define FLASH_FMC_ERASE (1u << 1)
#define FLASH_FCRIS LM3S_REG(0x400FD00Cu)
#define FLASH_FCMISC LM3S_REG(0x400FD014u)
#define FLASH_FCRIS_ARIS (1u << 0) /* access (protection) violation */

/* ---- Cortex-M3 core ---- */
#define SYST_CSR LM3S_REG(0xE000E010u)
#define SYST_CSR_ENABLE (1u << 0)
#define SYST_CSR_TICKINT (1u << 1)
#define SYST_CSR_CLKSOURCE (1u << 2) /* processor clock */
#define SYST_RVR LM3S_REG(0xE000E014u)
#define SYST_CVR LM3S_REG(0xE000E018u)
#define NVIC_ISER(n) LM3S_REG(0xE000E100u + 4u * (n))
#define NVIC_ICER(n) LM3S_REG(0xE000E180u + 4u * (n))

static inline void lm3s_irq_disable(void) { __asm__ volatile("cpsid i" ::: "memory"); }
static inline void lm3s_irq_enable(void) { __asm__ volatile("cpsie i" ::: "memory"); }
static inline void lm3s_wfi(void) { __asm__ volatile("wfi" ::: "memory"); }

#endif /* ODOLINK_LM3S6965_H_ */
