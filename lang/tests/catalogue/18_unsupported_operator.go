// Only + - * / are available in conditions.
package Modulo

var D1 Quadcopter

func INIT() {
	WaitUntil(D1.X() % 2 == 0, SEQ_Land)
}

func SEQ_Land() {
	D1.Land()
}
